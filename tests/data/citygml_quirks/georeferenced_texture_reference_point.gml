<?xml version="1.0" encoding="UTF-8"?>
<!-- cityatlas test fixture, hand-written (GPL-3.0-or-later). The roof is textured by a GeoreferencedTexture placed by referencePoint + orientation (2.5 m x 2 m pixels, upper left pixel centre at the roof corner). -->
<CityModel xmlns="http://www.opengis.net/citygml/2.0" xmlns:gml="http://www.opengis.net/gml" xmlns:bldg="http://www.opengis.net/citygml/building/2.0" xmlns:app="http://www.opengis.net/citygml/appearance/2.0" xmlns:xlink="http://www.w3.org/1999/xlink" xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:schemaLocation="http://www.opengis.net/citygml/2.0 http://schemas.opengis.net/citygml/profiles/base/2.0/CityGML.xsd">
  <gml:boundedBy>
    <gml:Envelope srsName="urn:ogc:def:crs:EPSG::25832" srsDimension="3">
      <gml:lowerCorner>690000.0 5336000.0 500.0</gml:lowerCorner>
      <gml:upperCorner>690030.0 5336008.0 506.0</gml:upperCorner>
    </gml:Envelope>
  </gml:boundedBy>
  <cityObjectMember>
    <bldg:Building gml:id="B_georef">
      <bldg:boundedBy>
        <bldg:GroundSurface gml:id="B_georef_ground_surface">
          <bldg:lod2MultiSurface>
            <gml:MultiSurface>
              <gml:surfaceMember>
                <gml:Polygon gml:id="B_georef_ground">
                  <gml:exterior>
                    <gml:LinearRing gml:id="B_georef_ground_ring">
                      <gml:posList srsDimension="3">690000.00 5336000.00 500.00 690000.00 5336008.00 500.00 690010.00 5336008.00 500.00 690010.00 5336000.00 500.00 690000.00 5336000.00 500.00</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Polygon>
              </gml:surfaceMember>
            </gml:MultiSurface>
          </bldg:lod2MultiSurface>
        </bldg:GroundSurface>
      </bldg:boundedBy>
      <bldg:boundedBy>
        <bldg:WallSurface gml:id="B_georef_wall_s_surface">
          <bldg:lod2MultiSurface>
            <gml:MultiSurface>
              <gml:surfaceMember>
                <gml:Polygon gml:id="B_georef_wall_s">
                  <gml:exterior>
                    <gml:LinearRing gml:id="B_georef_wall_s_ring">
                      <gml:posList srsDimension="3">690000.00 5336000.00 500.00 690010.00 5336000.00 500.00 690010.00 5336000.00 506.00 690000.00 5336000.00 506.00 690000.00 5336000.00 500.00</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Polygon>
              </gml:surfaceMember>
            </gml:MultiSurface>
          </bldg:lod2MultiSurface>
        </bldg:WallSurface>
      </bldg:boundedBy>
      <bldg:boundedBy>
        <bldg:WallSurface gml:id="B_georef_wall_e_surface">
          <bldg:lod2MultiSurface>
            <gml:MultiSurface>
              <gml:surfaceMember>
                <gml:Polygon gml:id="B_georef_wall_e">
                  <gml:exterior>
                    <gml:LinearRing gml:id="B_georef_wall_e_ring">
                      <gml:posList srsDimension="3">690010.00 5336000.00 500.00 690010.00 5336008.00 500.00 690010.00 5336008.00 506.00 690010.00 5336000.00 506.00 690010.00 5336000.00 500.00</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Polygon>
              </gml:surfaceMember>
            </gml:MultiSurface>
          </bldg:lod2MultiSurface>
        </bldg:WallSurface>
      </bldg:boundedBy>
      <bldg:boundedBy>
        <bldg:WallSurface gml:id="B_georef_wall_n_surface">
          <bldg:lod2MultiSurface>
            <gml:MultiSurface>
              <gml:surfaceMember>
                <gml:Polygon gml:id="B_georef_wall_n">
                  <gml:exterior>
                    <gml:LinearRing gml:id="B_georef_wall_n_ring">
                      <gml:posList srsDimension="3">690010.00 5336008.00 500.00 690000.00 5336008.00 500.00 690000.00 5336008.00 506.00 690010.00 5336008.00 506.00 690010.00 5336008.00 500.00</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Polygon>
              </gml:surfaceMember>
            </gml:MultiSurface>
          </bldg:lod2MultiSurface>
        </bldg:WallSurface>
      </bldg:boundedBy>
      <bldg:boundedBy>
        <bldg:WallSurface gml:id="B_georef_wall_w_surface">
          <bldg:lod2MultiSurface>
            <gml:MultiSurface>
              <gml:surfaceMember>
                <gml:Polygon gml:id="B_georef_wall_w">
                  <gml:exterior>
                    <gml:LinearRing gml:id="B_georef_wall_w_ring">
                      <gml:posList srsDimension="3">690000.00 5336008.00 500.00 690000.00 5336000.00 500.00 690000.00 5336000.00 506.00 690000.00 5336008.00 506.00 690000.00 5336008.00 500.00</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Polygon>
              </gml:surfaceMember>
            </gml:MultiSurface>
          </bldg:lod2MultiSurface>
        </bldg:WallSurface>
      </bldg:boundedBy>
      <bldg:boundedBy>
        <bldg:RoofSurface gml:id="B_georef_roof_surface">
          <bldg:lod2MultiSurface>
            <gml:MultiSurface>
              <gml:surfaceMember>
                <gml:Polygon gml:id="B_georef_roof">
                  <gml:exterior>
                    <gml:LinearRing gml:id="B_georef_roof_ring">
                      <gml:posList srsDimension="3">690000.00 5336000.00 506.00 690010.00 5336000.00 506.00 690010.00 5336008.00 506.00 690000.00 5336008.00 506.00 690000.00 5336000.00 506.00</gml:posList>
                    </gml:LinearRing>
                  </gml:exterior>
                </gml:Polygon>
              </gml:surfaceMember>
            </gml:MultiSurface>
          </bldg:lod2MultiSurface>
        </bldg:RoofSurface>
      </bldg:boundedBy>
    </bldg:Building>
  </cityObjectMember>
  <app:appearanceMember>
    <app:Appearance>
      <app:theme>rgbTexture</app:theme>
      <app:surfaceDataMember>
        <app:GeoreferencedTexture gml:id="TEX_georeferenced">
          <app:imageURI>tex/facade.png</app:imageURI>
          <app:mimeType>image/png</app:mimeType>
          <app:referencePoint>
            <gml:Point>
              <gml:pos srsDimension="2">690000.00 5336008.00</gml:pos>
            </gml:Point>
          </app:referencePoint>
          <app:orientation>2.5 0.0 0.0 -2.0</app:orientation>
          <app:target>#B_georef_roof</app:target>
        </app:GeoreferencedTexture>
      </app:surfaceDataMember>
    </app:Appearance>
  </app:appearanceMember>
</CityModel>
